"""Physics: the world as data, and the PyBullet world that flies the vehicle body in it.

Importing this package does not load pybullet; `pybullet_world` and `scene` do."""
