"""The ``enc`` commands: one thin module per command over the library."""
