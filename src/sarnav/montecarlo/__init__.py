"""sarnav.montecarlo"""
