# ROS targets are added here in a later step
