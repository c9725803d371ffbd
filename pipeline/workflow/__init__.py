"""User-facing specs (YAML, pydantic) converted to plain arguments for the stages."""
