"""The physics of the lumped-mass model: the simulation, its identification, the named effects."""
