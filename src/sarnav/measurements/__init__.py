"""sarnav.measurements"""
