"""The host's contour controllers (cross-coupled, variable-gain cross-coupled, contour error
controller) and the path geometry they need: plain Python host firmware."""
