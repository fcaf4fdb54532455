"""The shape and what every stage needs of it: the validating Mesh, topology, repair of a private copy,
transforms and rotations, the sparse solver, progress, mesh reports, the up axis."""
