"""The world the vehicle moves in: ocean flow, the dock and the truth plant."""
