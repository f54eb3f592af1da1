"""sarnav.cli"""
