"""sarnav.filters"""
