"""Where runs are stored unless the user names a database."""

#: SQLite file in the working directory; any SQLAlchemy URL (e.g. PostgreSQL) works too.
DEFAULT_URL = "sqlite:///colloc-runs.db"
