"""rosbag2 MCAP bags: writer, MCAP file, reader, recovery, metadata YAML, time response."""
