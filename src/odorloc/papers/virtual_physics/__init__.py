"""Paper package."""
