"""sarnav.ins"""
