"""Deformation: cage ARAP, the selection model, propagation with the residual, exact constraints, the region
step, the pose an edit starts from, the polish, the limb skeleton and the limbs found on it, the record of
a pose and its replay, and the editor (the engine's front door, editor.py) with the parts it is made of (role_queries,
editor_state, recorded_edits, editor_files, limb_posing) and the arguments it takes (transform_arguments,
rig_arguments)."""
