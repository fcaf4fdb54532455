"""The control mesh: quadric simplification (on two cores for big shapes), one closed piece per part, thin
shells around sheets, links between pieces."""
