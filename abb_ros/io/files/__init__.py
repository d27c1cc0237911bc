"""The files the package reads: scenarios, drive and map files, their fields, safe YAML."""
