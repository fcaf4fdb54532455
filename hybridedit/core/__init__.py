"""The shape and what every stage needs of it: the validating Mesh, topology, repair of a private copy,
face geometry and normals, ARAP edge weights, transforms and rotations, the sparse solver, progress,
mesh reports, the up axis's guess, and the small rules every floor shares (the shape fingerprint, the
cache folder, the commands' arguments)."""
