"""The job queue: SQLite store, supervisor of isolated job processes (upload checks: intake)."""
