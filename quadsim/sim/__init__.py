"""The simulation: the run's settings, the loop that owns the clock, each vehicle (a Drone) and
the fleet that steps them on one clock (a Simulator is the fleet of one)."""
