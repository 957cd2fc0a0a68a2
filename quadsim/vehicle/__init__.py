"""The vehicle model: parameters read from the URDF and its parameter file, the mixer, the motors."""
