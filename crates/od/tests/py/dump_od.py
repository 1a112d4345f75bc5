"""Dump what python-canopen's import_od reads from EDS/DCF files, for the cross-check test.

For every file given on the command line, print one line per variable:
    FILE <TAB> index <TAB> subindex <TAB> data_type <TAB> access_type <TAB> pdo_mappable(0/1)
or, when python-canopen cannot read the file:
    FILE <TAB> ERROR <TAB> exception type and message
Files that are not UTF-8 are retried as Latin-1 (python-canopen opens files with the locale
encoding), and a line "FILE <TAB> NOTE <TAB> latin-1" says so.
"""
import sys

import canopen
from canopen.objectdictionary import ODArray, ODRecord, ODVariable


def rows(od):
    for obj in od.values():
        if isinstance(obj, ODVariable):
            yield obj
        elif isinstance(obj, (ODArray, ODRecord)):
            for var in obj.values():
                yield var


def dump(path):
    try:
        try:
            od = canopen.import_od(path)
        except UnicodeDecodeError:
            print(f"{path}\tNOTE\tlatin-1")
            with open(path, encoding="latin-1") as fp:
                od = canopen.import_od(fp)
    except Exception as e:  # noqa: BLE001 - report every failure of the other parser
        msg = str(e).replace("\n", " ").replace("\t", " ")
        print(f"{path}\tERROR\t{type(e).__name__}: {msg}")
        return
    seen = set()
    for var in rows(od):
        key = (var.index, var.subindex)
        if key in seen:
            continue
        seen.add(key)
        print(f"{path}\t{var.index}\t{var.subindex}\t{var.data_type}\t{var.access_type}\t{int(bool(var.pdo_mappable))}")


def main():
    for path in sys.argv[1:]:
        dump(path)


if __name__ == "__main__":
    main()
