"""Reporting: tables and plots (matplotlib); no computation."""
