"""A mass-spring-damper written as a vectorid model of your own (see dynamics.py)."""
