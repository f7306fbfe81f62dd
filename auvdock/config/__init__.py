"""Input files: missions, their schema, strict YAML and the shipped catalogue."""
