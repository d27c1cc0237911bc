"""Pure physics of the drive (numpy/scipy and a compiled kernel); no ROS imports here."""
