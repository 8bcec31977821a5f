"""fic_teleop_bringup: starts the fic_teleop graph (the launcher), with the differences between run modes as YAML
run profiles (../profiles), and the two-station deployment. docs/ARCHITECTURE.md, "Bringup"."""
