"""
Quickstart
==========

placeholder
"""

print("hi")
