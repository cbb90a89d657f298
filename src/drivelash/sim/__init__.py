"""Closed-loop drive-train simulation: engine, sensor model and named scenarios."""
