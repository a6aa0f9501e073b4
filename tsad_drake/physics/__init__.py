"""The physics world: pick-and-places executed as Drake contact simulations (issue 19)."""
