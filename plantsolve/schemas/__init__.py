"""Pydantic models of every request and result: the one contract shared by the API,
the CLI, the workers and the OpenAPI document.

This package imports nothing from the rest of plantsolve.
"""
