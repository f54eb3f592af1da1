"""sarnav.analysis"""
