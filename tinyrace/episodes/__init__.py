"""Episodes per track kind: the rules, reading the world's contacts, car states and track.

An episode steps its ``World`` (``tinyrace/world``) and turns what happened into
``StepFacts`` (tiles visited, laps, bounds, obstacle colours, cte); it draws nothing
(pictures live in ``tinyrace/render``).

``episodes/setup.py`` turns a loaded config into the env's parts (car model, track
source, course); a course makes one episode per reset.
"""
