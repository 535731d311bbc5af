"""Episodes: the rules, reading the world's contacts, car states and track.

An episode (``episode.py``) steps its ``World`` (``tinyrace/world``) and turns what
happened into each car's ``StepFacts`` (tiles visited, laps, bounds, obstacle colours,
collisions, cte) through the rule parts its track lists (``rules.py``); it draws
nothing (pictures live in ``tinyrace/render``).

``setup.py`` turns a loaded config into the env's parts (car model, track source,
course); the course makes one episode per reset.
"""
