#!/usr/bin/env bash
# Regenerates plate-with-hole.msh and re-entrant-corner.msh (ASCII MSH 2.2, all quads) from the .geo files.
# gmsh is the Debian package gmsh, needed only to regenerate: the .msh files are committed.
set -e
cd "$(dirname "$0")"
gmsh -2 -format msh22 plate-with-hole.geo -o plate-with-hole.msh
gmsh -2 -format msh22 re-entrant-corner.geo -o re-entrant-corner.msh
