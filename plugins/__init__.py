"""Built-in psdr-room plugins."""
