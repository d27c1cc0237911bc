"""What the drive's sensors read: sampling schedule, IMU, FG speed sensor, faults, disturbances."""
