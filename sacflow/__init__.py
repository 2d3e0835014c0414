"""sacflow."""
