"""One module per `deflare-scene` command, each with ``register(app)`` (workflows/cli.py)."""
