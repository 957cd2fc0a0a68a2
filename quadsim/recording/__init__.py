"""Recording: the ROS 2 topic contract, the MCAP writer and reader, salvage and info."""
