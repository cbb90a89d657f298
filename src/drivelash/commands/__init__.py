"""CLI command modules; each defines ``register(app, te_app)``."""
