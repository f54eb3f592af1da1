"""sarnav.sensors"""
