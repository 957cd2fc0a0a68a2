"""The simulation: the run's settings, the loop that owns the clock, and the assembled Simulator."""
