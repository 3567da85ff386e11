"""Fetches the headers of an OpenUSD release (what cpp-bridge/hydra/check_headers.sh needs:
pxr/**/*.h, pxr/pxr.h.in and cmake/defaults/Version.cmake) into a directory, from the
release's source archive on GitHub, without building anything.

    python scripts/fetch_openusd_headers.py TAG DEST [--archive FILE_OR_URL]

TAG is a release tag (v24.08); DEST receives pxr/ and cmake/ (written to a temporary
directory beside it and renamed into place, so DEST is whole or absent). --archive reads
another .tar.gz (a local file or URL) laid out as GitHub's archives are (one top directory).
Exit status: 0 when DEST holds the headers, 1 when the archive cannot be had or holds none."""
import argparse
import os
import shutil
import sys
import tarfile
import tempfile
import urllib.request

WANTED_SUFFIXES = (".h",)
WANTED_FILES = ("pxr/pxr.h.in", "cmake/defaults/Version.cmake")


def wanted(path):
    """Whether an archive member (its path below the top directory) is one the check reads."""
    return path in WANTED_FILES or (path.startswith("pxr/") and path.endswith(WANTED_SUFFIXES))


def extract(stream, dest):
    """Extracts the wanted members of the gzipped tar `stream` into `dest`; returns how many."""
    count = 0
    with tarfile.open(fileobj=stream, mode="r|gz") as tar:
        for member in tar:
            parts = member.name.split("/", 1)
            if len(parts) < 2 or not member.isfile() or not wanted(parts[1]):
                continue
            inner = os.path.normpath(parts[1])
            if inner.startswith("..") or os.path.isabs(inner):
                continue
            target = os.path.join(dest, inner)
            os.makedirs(os.path.dirname(target), exist_ok=True)
            src = tar.extractfile(member)
            with open(target, "wb") as out:
                shutil.copyfileobj(src, out)
            count += 1
    return count


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tag")
    ap.add_argument("dest")
    ap.add_argument("--archive", help="a .tar.gz file or URL instead of the release's archive")
    args = ap.parse_args(argv)
    source = args.archive or \
        "https://github.com/PixarAnimationStudios/OpenUSD/archive/refs/tags/%s.tar.gz" % args.tag
    dest = os.path.abspath(args.dest)
    parent = os.path.dirname(dest)
    os.makedirs(parent, exist_ok=True)
    work = tempfile.mkdtemp(prefix=".openusd-headers-", dir=parent)
    try:
        if os.path.exists(source):
            with open(source, "rb") as f:
                count = extract(f, work)
        else:
            with urllib.request.urlopen(source, timeout=60) as r:
                count = extract(r, work)
        if count == 0 or not all(os.path.isfile(os.path.join(work, f)) for f in WANTED_FILES):
            print("fetch_openusd_headers: %s holds no OpenUSD headers" % source, file=sys.stderr)
            return 1
        if os.path.exists(dest):
            shutil.rmtree(dest)
        os.rename(work, dest)
        work = None
        print("fetch_openusd_headers: %d files of %s in %s" % (count, args.tag, dest))
        return 0
    except (OSError, tarfile.TarError) as e:
        print("fetch_openusd_headers: cannot read %s: %s" % (source, e), file=sys.stderr)
        return 1
    finally:
        if work:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
