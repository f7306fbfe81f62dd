"""Hardware: ArduSub's thrust path (:mod:`.ardusub`) for flying a real BlueROV2 over MAVLink."""
