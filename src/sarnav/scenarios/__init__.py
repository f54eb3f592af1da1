"""sarnav.scenarios"""
