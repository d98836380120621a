"""The built-in psdr-room plugins: each module or package is one entry point of group ``psdr_room``
(``pyproject.toml``), registering implementations of the method's capabilities as a third party would."""
