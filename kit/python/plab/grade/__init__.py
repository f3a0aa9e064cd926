"""plab.grade: the autograder (`python3 -m plab.grade`, what `plab grade` runs) and its parts, one
module per concern:

  __main__     the options (declared here only) and one grading or a class's
  grader       Grader: one grading, made of the mixins below, the sandbox chosen, the stages run
  stage        the rubric's graded entries; the refusal to grade
  results      results.json (Gradescope's format, its leaderboard included) and JUnit XML
  build        the submission's stages built with the kit's own code in the sandbox
  run          student code run in the sandbox; the reference's outputs; verdict and diagnosis
  correctness  public and hidden scenes, one step at a time
  ideas        each stage's idea, measured outside its code
  racecheck    the data-race test (ThreadSanitizer; races: its build, environment and report)
  performance  the timed runs against the reference
  leaderboard  the measured times, relative scoring, the class's leaderboard page
  hidden       the hidden scenes of a grading's seed (checked with the reference's --json events)
  sandbox      bubblewrap or an unprivileged user, limits
  upload       what a student uploaded, found and checked
  classroom    a class graded in one command (--class)
  race_check   `plab test --races`: the race check without the sandbox
  release      `plab release`: the student copy of the kit
  gradescope   `plab gradescope`: the autograder zip
"""
