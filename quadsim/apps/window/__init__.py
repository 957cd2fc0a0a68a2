"""The desktop window (pygame): teleop and replay share one view."""
