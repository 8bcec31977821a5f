"""Recording: the rosbag2-layout MCAP writer, the one sequential reader (which also reads a torn bag), the
recovery of a torn bag, and the recorder node."""
