"""The rubric's graded entries (Stage) and the grader's refusal to grade (Refused)."""



class Refused(Exception):
    """The grader will not grade (no sandbox, a private file readable, a stage it does not know):
    the text says why and what to do."""


class Stage:
    """One graded entry of the rubric: a stage folder of the kit, on a device, against a
    reference. `key` is the rubric's name ("06", "06-gpu"), `sid` the folder's number."""

    def __init__(self, key, conf, manifest):
        self.key, self.conf = key, conf
        self.sid = conf.get("folder", key)
        self.gpu = conf.get("gpu", False)
        self.threads = str(conf.get("threads", 1))
        self.reference = conf.get("reference", manifest["reference_stage"])
        # whose text a student copy's compiled reference program (kit/reference/bin) prints
        self.released_reference = self.reference == manifest["reference_stage"]
        self.exact = conf.get("golden") == "exact"
        self.env = {"PLAB_DEVICE": conf["device"]} if "device" in conf else {}
        self.ranks = int(conf.get("ranks", 1))  # a stage on several processes: mpirun starts them
        self.idea = conf.get("idea")  # the stage's idea test (Grader.idea_test), or None
        self.title = f"stage {key}"
