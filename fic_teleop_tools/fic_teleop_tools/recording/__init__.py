"""Recording: the rosbag2-layout MCAP writer, the one sequential reader (which also reads a torn bag), the
recovery of a torn bag, the recorder node, and the live view it serves (live_view.py) with the Foxglove layout
of it (live_view_layout.py)."""
