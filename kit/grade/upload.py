"""What a student uploaded, as `plab grade` finds it: the kit folder, a `stages/` folder, a zip of
either, or one stage's files flat (taken when their banner names the stage, or when one stage is
asked for). Anything else is a short message naming what was found and what is expected.
"""
import pathlib
import re
import shutil
import stat
import zipfile

SOURCES = (".cpp", ".hpp", ".h", ".cu", ".cuh")  # what is taken from a submission's stage
ZIP_LIMIT = 64 * 2**20  # bytes an upload's zip may unpack to
EXPECTED = ("expected: the kit folder (with stages/NN-name/), a stages/ folder, a zip of either, "
            "or one stage's files (step.cpp ...) with their '\\file stages/NN-name/...' banner")


class UploadError(Exception):
    """An upload the grader cannot take; its text is the message for the student (3 lines)."""


def sources(folder):
    """The source files of a stage folder (no links, no sub-folders)."""
    return sorted(p for p in folder.iterdir()
                  if p.suffix in SOURCES and p.is_file() and not p.is_symlink())


def _unzip(archive, dest):
    """Unpacks a zip safely: no absolute paths, no '..', no links, at most ZIP_LIMIT bytes."""
    total = 0
    with zipfile.ZipFile(archive) as z:
        for info in z.infolist():
            name = pathlib.PurePosixPath(info.filename)
            if name.is_absolute() or ".." in name.parts or "__MACOSX" in name.parts:
                continue
            if stat.S_ISLNK(info.external_attr >> 16):
                continue
            total += info.file_size
            if total > ZIP_LIMIT:
                raise UploadError(f"the zip {archive.name} unpacks to more than "
                                  f"{ZIP_LIMIT // 2**20} MB\n{EXPECTED}\nupload only your stages/")
            target = dest / name
            if info.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            with z.open(info) as src, open(target, "wb") as out:
                shutil.copyfileobj(src, out)
    return dest


def _stage_folders(root, kit_folders):
    """{stage id: folder} of the kit's stage folder names found directly in `root`."""
    return {sid: root / name for sid, name in kit_folders.items() if (root / name).is_dir()}


def _banner_stage(path, kit_folders):
    """The stage a source file's banner names ('\\file stages/01-naive/step.cpp'), or None."""
    head = path.read_text(errors="replace")[:400]
    m = re.search(r"\\file\s+(?:stages|solutions)/(\d\d)-", head)
    return m.group(1) if m and m.group(1) in kit_folders else None


def _describe(root):
    names = sorted(p.name + ("/" if p.is_dir() else "") for p in root.iterdir())
    return ", ".join(names[:8]) + (" ..." if len(names) > 8 else "") if names else "nothing"


def find_stages(submission, kit_folders, wanted, scratch):
    """Locates the stages in an upload. `kit_folders`: {id: folder name} of the kit; `wanted`:
    stage ids asked for (empty: whatever the upload has). Returns ({id: folder with the
    sources}, a note saying what layout was taken)."""
    root = pathlib.Path(submission)
    if root.is_file() and root.suffix == ".zip":
        root = _unzip(root, scratch / "upload")
    zips = [p for p in root.iterdir() if p.suffix == ".zip"] if root.is_dir() else []
    if root.is_dir() and len(zips) == 1 and not _stage_folders(root / "stages", kit_folders):
        others = [p for p in root.iterdir() if p != zips[0] and not p.name.startswith(".")]
        if not others:
            root = _unzip(zips[0], scratch / "upload")
            note = f"unpacked {zips[0].name}; "
        else:
            note = ""
    else:
        note = ""
    # A single folder at the top (a zip of the kit folder, a folder uploaded whole): go in.
    for _ in range(2):
        entries = [p for p in root.iterdir() if not p.name.startswith((".", "__MACOSX"))]
        if len(entries) == 1 and entries[0].is_dir() and not _stage_folders(root, kit_folders):
            root = entries[0]
    for candidate, layout in ((root / "stages", "the kit's stages/ folder"),
                              (root, "a stages/ folder")):
        found = _stage_folders(candidate, kit_folders)
        if found:
            return found, note + f"took {layout}: stages {', '.join(sorted(found))}"
    flat = sources(root)
    if flat:
        named = {s for s in (_banner_stage(p, kit_folders) for p in flat) if s}
        if len(named) == 1:
            stage = named.pop()
        elif not named and len(wanted) == 1:
            stage = wanted[0]
        else:
            which = f"stages {', '.join(sorted(named))}" if named else "no stage"
            raise UploadError(
                f"found {len(flat)} source files flat ({_describe(root)}) whose banners name {which}\n"
                f"{EXPECTED}\nor pass --stages NN to say which stage these files are")
        dest = scratch / "flat" / kit_folders[stage]
        dest.mkdir(parents=True)
        for p in flat:
            shutil.copy2(p, dest / p.name)
        return {stage: dest}, note + (f"took {len(flat)} files uploaded flat "
                                      f"({', '.join(p.name for p in flat)}) as stage {stage}")
    raise UploadError(f"found {_describe(root)}: no stage folder and no source file\n{EXPECTED}\n"
                      "re-upload your stages/ folder (or the whole kit folder)")
