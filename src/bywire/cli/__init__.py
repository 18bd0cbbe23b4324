"""Command-line interface: thin wrappers that parse, load and call."""
