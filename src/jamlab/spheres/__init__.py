"""Soft spheres: Lees–Edwards box, cell lists, harmonic potential, FIRE, packings, AQS shear."""
