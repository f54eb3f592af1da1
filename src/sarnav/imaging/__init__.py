"""sarnav.imaging"""
