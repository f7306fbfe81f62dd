"""The closed loop: the autopilot step (estimation + control) and the loop that runs it."""
