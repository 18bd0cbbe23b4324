"""`bywire monitor`: a live, decoded view of any CAN bus (model, view, feed and the app)."""
