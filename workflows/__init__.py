"""The deflare-scene command line and its compositions of stages (product and research)."""
