"""The flight's data types and kinematics helpers: plain Python, no pybullet, pygame or numpy."""
