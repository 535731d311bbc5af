"""Episodes per track kind: what a step does on the world and which facts it reports.

``episodes/setup.py`` turns a loaded config into the env's parts (car model, track
source, course); a course makes one episode per reset.
"""
