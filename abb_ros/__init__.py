"""abb_ros: an optical disk drive with an automatic ball balancer, as a ROS 2 plant."""
