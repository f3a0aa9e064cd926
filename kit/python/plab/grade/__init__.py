"""plab.grade: the autograder (`python3 -m plab.grade`, what `plab grade` runs) and its parts:
the sandbox, the hidden scenes, the race check, uploads, a class's batch, the student release and
the Gradescope bundle."""
