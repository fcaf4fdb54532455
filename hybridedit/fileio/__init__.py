"""Files: meshes (a module per format behind one registry), the document that keeps everything a file holds,
edit files, output paths checked before any work, atomic writes, the up axis remembered per shape, the user's
one-time flags (a hint dismissed)."""
