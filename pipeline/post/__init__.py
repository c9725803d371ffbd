"""Post-processing: off-screen renders (pyvista), plots (matplotlib), exports."""
