"""Judging a run's FDI against its ground truth, without ROS: the evaluation figures (metrics) and a recorded
run read back as what they take (bag_series). ``rw-fdi run``'s verdict, screen, evaluate and every bench
score runs here."""
