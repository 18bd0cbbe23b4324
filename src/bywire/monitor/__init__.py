"""`bywire monitor`: a live, decoded view of any CAN bus (model, view, bus_reader and the app)."""
