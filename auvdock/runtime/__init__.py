"""What the loop runs on: the injected clock, Ctrl-C handling, compiled CasADi code, step timing."""
