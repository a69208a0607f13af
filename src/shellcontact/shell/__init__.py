"""The Kirchhoff-Love cylindrical shell: geometry, material, mesh, P2 x P2 x Argyris spaces, strains
and stiffness (model), edge conditions (supports) and loads.
"""
