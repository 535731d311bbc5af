"""Episodes: the step of every car, owned once, judged by rule parts.

An episode (``episode.py``) steps its ``World`` (``tinyrace/world``), turns what happened
into each car's ``StepFacts`` (tiles visited, laps, bounds, obstacle colours, collisions,
cte) through the rule parts its track lists (``rules/``, one module each), keeps the
clock, the step counter and the scores, and has its ``Referee`` (``referee.py``) judge
each car: reward terms, reward, end, truncation. It draws nothing (pictures live in
``tinyrace/render``).

``setup.py`` turns a loaded config into the env's parts (car model, track source,
course); the course makes one episode per reset.
"""
