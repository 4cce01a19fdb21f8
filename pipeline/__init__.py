"""The deflare-scene stages (one module each) and the workspace contract they share."""
