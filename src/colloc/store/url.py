"""Where runs are stored unless the user names a database."""

DEFAULT_URL = "sqlite:///colloc-runs.db"
"""SQLite file in the working directory; any SQLAlchemy URL (e.g. PostgreSQL) works too."""
