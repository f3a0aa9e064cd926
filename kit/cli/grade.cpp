/// \file cli/grade.cpp
/// \brief `plab grade`: the autograder.
#include "common.hpp"

namespace plab::cli {

void add_grade(CLI::App& app) {
  struct Args {
    std::string submission, klass, stages, out, junit, rubric, scratch;
    int jobs = 0;
    bool regrade = false;
    std::string sandbox = "auto";
    long long seed = -1;
    bool keep = false, no_sandbox = false, make_private = false, races = false, no_races = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "grade", "Grade a submission: builds its stages with the kit's own code in a sandbox, runs "
               "them there under limits against public and hidden scenes, one step at a time and "
               "for speed, and writes Gradescope's results.json, JUnit XML and a summary (with the "
               "hidden scenes' seed). Points: kit/grade/rubric.json.");
  auto* one = c->add_option("--submission", a->submission,
                            "what the student uploaded: the kit folder, a stages/ folder, a zip of "
                            "either, or one stage's files flat")
                  ->check(CLI::ExistingPath);
  auto* many = c->add_option("--class", a->klass,
                             "grade a class: a folder with one submission (folder or zip) per "
                             "student, each in its own sandbox; writes OUT/gradebook.csv, "
                             "OUT/summary.html and OUT/students/NAME/results.json (resumable)")
                   ->check(CLI::ExistingDirectory);
  one->excludes(many);
  c->add_option("--jobs", a->jobs,
                "with --class: submissions graded at a time (default: one per two cores)")
      ->check(CLI::PositiveNumber);
  c->add_flag("--regrade", a->regrade,
              "with --class: grade again the submissions already graded (default: resume)");
  c->add_option("--stages", a->stages,
                "stages to grade, e.g. 01,06 (default: every stage the submission has; 06 means "
                "06 on the CPU and, with a GPU, 06-gpu)");
  c->add_option("--out", a->out, "results.json to write (default results.json; always written; "
                                 "the summary goes beside it, NAME.summary.txt); with --class, "
                                 "the folder of the class's results (default grades)");
  c->add_option("--junit", a->junit, "JUnit XML to write (default: beside --out, .xml)");
  c->add_option("--seed,--hidden-seed", a->seed,
                "the hidden scenes' seed: replays a grading (default: random, recorded in the "
                "summary and in results.json's extra_data)");
  c->add_option("--rubric", a->rubric, "rubric file (default: kit/grade/rubric.json)");
  c->add_option("--scratch", a->scratch, "where to build and run (default: the system's temp)");
  c->add_option("--sandbox", a->sandbox,
                "auto (bubblewrap where namespaces are allowed, else an unprivileged user), "
                "bwrap or user")
      ->check(CLI::IsMember({"auto", "bwrap", "user"}))->capture_default_str();
  c->add_flag("--no-sandbox", a->no_sandbox,
              "run student code with the grader's own rights (printed on every result)");
  c->add_flag("--keep", a->keep, "keep the scratch folder");
  c->add_flag("--make-private", a->make_private,
              "with the unprivileged-user sandbox (no namespaces): take group and other "
              "permissions from the kit's answers (solutions, goldens, build) before grading; "
              "without it the grader refuses while they are readable");
  c->add_flag("--races", a->races,
              "(the default) build the stages whose rubric marks races (03, 06) again with "
              "ThreadSanitizer in the sandbox and report the first data race with file and line");
  c->add_flag("--no-races", a->no_races,
              "skip the ThreadSanitizer check (its points are then not given)");
  c->callback([a] {
    if (default_impl() != "solution")
      throw std::runtime_error("grading needs the instructor's kit (with solutions/)");
    if (a->submission.empty() == a->klass.empty())
      throw std::runtime_error("grade: give --submission (one student) or --class (a folder of "
                               "them)");
    std::vector<std::string> args{"python3", source_dir() + "/kit/grade/grade.py", "--rubric",
                                  a->rubric.empty() ? source_dir() + "/kit/grade/rubric.json"
                                                    : a->rubric,
                                  "--kit-source", source_dir(), "--kit-build", build_dir(),
                                  "--sandbox", a->sandbox};
    if (!a->stages.empty()) args.insert(args.end(), {"--stages", a->stages});
    if (!a->junit.empty()) args.insert(args.end(), {"--junit", a->junit});
    // The seed goes through the environment, which other users cannot read (a command line
    // can be read by every process of the machine, student code run as another uid included).
    if (a->seed >= 0) setenv("PLAB_GRADE_SEED", std::to_string(a->seed).c_str(), 1);
    if (!a->scratch.empty()) args.insert(args.end(), {"--scratch", a->scratch});
    if (a->keep) args.emplace_back("--keep");
    if (a->no_sandbox) args.emplace_back("--no-sandbox");
    if (a->make_private) args.emplace_back("--make-private");
    if (a->races) args.emplace_back("--races");
    if (a->no_races) args.emplace_back("--no-races");
    if (!a->klass.empty()) {  // the class driver runs one grader a submission, J at a time
      std::vector<std::string> batch{"python3", source_dir() + "/kit/grade/classroom.py",
                                     "--class", a->klass, "--out",
                                     a->out.empty() ? "grades" : a->out};
      if (a->jobs > 0) batch.insert(batch.end(), {"--jobs", std::to_string(a->jobs)});
      if (a->regrade) batch.emplace_back("--regrade");
      batch.emplace_back("--");
      batch.insert(batch.end(), args.begin() + 2, args.end());
      g_status = run_program(batch);
      return;
    }
    args.insert(args.begin() + 2, {"--submission", a->submission, "--out",
                                   a->out.empty() ? "results.json" : a->out});
    g_status = run_program(args);
  });
}

}  // namespace plab::cli
