"""The typed scenario configuration, loaded from YAML with overrides and validated."""
