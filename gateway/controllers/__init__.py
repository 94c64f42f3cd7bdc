"""Thin HTTP controllers: parse the request, call one service, shape the response."""
