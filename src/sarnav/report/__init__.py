"""sarnav.report"""
