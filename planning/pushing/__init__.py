"""Fence pushes on convex polygons (Akella & Mason 1992); the public names are in :mod:`planning`."""
