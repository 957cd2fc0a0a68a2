"""Live bridges: the run's topics published as they happen, commands taken from outside."""
