"""sarnav.trajectory"""
