"""Stand-in vehicles: a MAVLink vehicle simulator and ArduPilot SITL's physics backend."""
