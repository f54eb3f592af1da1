"""sarnav.radar"""
