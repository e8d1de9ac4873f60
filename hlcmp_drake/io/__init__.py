"""Files in and out: demonstrations, skill files, run logs, atomic outputs, errors and
where the bundled models and scenarios live."""
