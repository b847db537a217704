"""Bridges between the working memory and the outside world."""
