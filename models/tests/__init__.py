"""Tests of the Python exporter (edgefusion_models). Run from the repository root:
    /usr/bin/python3 -m unittest discover -s models/tests -t models
"""
