"""Recipes: whole workflows as one call (data → encoder → training → evaluation), over the parts before them."""
