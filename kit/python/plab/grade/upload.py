"""What a student uploaded, as `plab grade` finds it: the kit folder, a `stages/` folder, a zip of
either, or one stage's files flat (taken when their banner names the stage, or when one stage is
asked for). Anything else is a short message naming what was found and what is expected.
"""
import os
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
    dest.mkdir(parents=True, exist_ok=True)  # a zip of nothing (or of links only) is an empty folder
    try:
        z = zipfile.ZipFile(archive)
    except (zipfile.BadZipFile, OSError) as e:
        raise UploadError(f"{archive.name} is not a zip that can be read ({e})\n{EXPECTED}\n"
                          "re-upload your stages/ folder (or a zip of it)")
    with z:
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


def _without_links(root, dest):
    """A copy of the folder `root` with every symbolic link left out (a link to a file or a
    folder: the kit's solutions/, say), read before anything else looks at the upload; only
    folders, sources and zips are copied. Returns (the copy, the links left out)."""
    dropped, total = [], 0
    dest.mkdir(parents=True)
    for here, dirs, files in os.walk(root, followlinks=False):
        rel = pathlib.Path(here).relative_to(root)
        for name in list(dirs):
            if (pathlib.Path(here) / name).is_symlink() or name in ("build", ".git"):
                dirs.remove(name)
                if (pathlib.Path(here) / name).is_symlink():
                    dropped.append(str(rel / name))
                continue
            (dest / rel / name).mkdir()
        for name in files:
            path = pathlib.Path(here) / name
            if path.is_symlink():
                dropped.append(str(rel / name))
                continue
            if path.suffix not in SOURCES + (".zip",) or not path.is_file():
                continue
            total += path.stat().st_size
            if total > ZIP_LIMIT:
                raise UploadError(f"the upload holds more than {ZIP_LIMIT // 2**20} MB of sources"
                                  f"\n{EXPECTED}\nupload only your stages/")
            shutil.copyfile(path, dest / rel / name)
    return dest, dropped


def _stage_folders(root, kit_folders):
    """{stage id: folder} of the kit's stage folder names found directly in `root`."""
    return {sid: root / name for sid, name in kit_folders.items() if (root / name).is_dir()}


def _banner_stage(path, kit_folders):
    """The stage a source file's banner names ('\\file stages/01-naive/step.cpp'), or None."""
    head = path.read_text(errors="replace")[:400]
    m = re.search(r"\\file\s+(?:stages|solutions)/(\d\d)-", head)
    return m.group(1) if m and m.group(1) in kit_folders else None


def _describe_plain(root):
    """_describe() of a folder, its links left out (an upload's links are never followed)."""
    names = sorted(p.name + ("/" if p.is_dir() and not p.is_symlink() else "")
                   for p in root.iterdir() if not p.is_symlink())
    return ", ".join(names[:8]) + (" ..." if len(names) > 8 else "") if names else "nothing"


def _describe(root):
    names = sorted(p.name + ("/" if p.is_dir() else "") for p in root.iterdir())
    return ", ".join(names[:8]) + (" ..." if len(names) > 8 else "") if names else "nothing"


def find_stages(submission, kit_folders, wanted, scratch):
    """Locates the stages in an upload. `kit_folders`: {id: folder name} of the kit; `wanted`:
    stage ids asked for (empty: whatever the upload has). Returns ({id: folder with the
    sources}, a note saying what layout was taken)."""
    root = pathlib.Path(submission)
    uploaded = root  # what the student sent, named in a message (the copy holds sources only)
    dropped = []
    if root.is_dir():  # links dropped before anything reads the upload
        root, dropped = _without_links(root, scratch / "upload-copy")
    if root.is_file() and root.suffix == ".zip":
        root = _unzip(root, scratch / "upload")
    elif not root.is_dir():
        raise UploadError(f"found {root.name}, neither a folder nor a zip\n{EXPECTED}\n"
                          "re-upload your stages/ folder (or the whole kit folder)")
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
    if dropped:
        note += (f"left out {len(dropped)} symbolic link(s) ({', '.join(dropped[:4])}"
                 f"{' ...' if len(dropped) > 4 else ''}): upload the files themselves; ")
    top = root  # flat files are named from here: a folder gone into shows in the note
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
                f"found {len(flat)} source file{'s' if len(flat) != 1 else ''} flat "
                f"({_describe(root)}) whose banners name {which}\n"
                f"{EXPECTED}\nre-upload them in their stages/NN-name/ folder, or with the banner line "
                "the kit's file starts with (an instructor grading them by hand can pass --stages "
                "NN instead)")
        dest = scratch / "flat" / kit_folders[stage]
        dest.mkdir(parents=True)
        for p in flat:
            shutil.copy2(p, dest / p.name)
        where = ", ".join(str(p.relative_to(top)) for p in flat)  # an odd folder shows here
        files = "1 file" if len(flat) == 1 else f"{len(flat)} files"
        return {stage: dest}, note + f"took {files} uploaded flat ({where}) as stage {stage}"
    shown = uploaded if uploaded.is_dir() and root != uploaded and not any(root.iterdir()) else root
    uploads = [e for e in root.iterdir() if not e.name.startswith(".") and
               (e.is_dir() or e.suffix == ".zip")]
    several = ("\n(a folder of several students' uploads, one each, is graded with "
               "plab grade --class)" if len(uploads) > 1 else "")
    raise UploadError(f"found {_describe_plain(shown)}: no stage folder and no source file\n"
                      f"{EXPECTED}\n"
                      "re-upload your stages/ folder (or the whole kit folder)" + several)
