"""Operation handlers: pure functions from a request model to a response model."""
