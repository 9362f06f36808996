"""`driver calibrate`: a target material into both models' parameters (issue 12, point 3)."""
