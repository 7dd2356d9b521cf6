"""Tumbles of convex polyhedra (Marigo & Bicchi); the public names are in :mod:`planning`."""
