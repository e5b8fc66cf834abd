"""Which packages the wheel holds: found automatically under each source folder.

drivers/ and simulators/ stay top-level folders but install as ``ecds_lab.drivers`` and
``ecds_lab.simulators`` (no generic top-level import name lands in site-packages), and
experiments/ installs as ``ecds_lab.experiments``: its YAML is package data, its sub-folders
(stations/, sensors/) data-only namespace packages. setuptools' ``find`` cannot add a name
prefix, so the prefix is added here; everything else is in pyproject.toml.
"""

from setuptools import find_namespace_packages, find_packages, setup

#: Import name -> source folder. Every package below a folder is found and installed under its name.
ROOTS = {
    "ecds_lab": "ecds_lab",
    "ecds_lab.drivers": "drivers",
    "ecds_lab.simulators": "simulators",
}
#: Import name -> folder of shipped data files (YAML), every sub-folder included.
DATA_ROOTS = {"ecds_lab.experiments": "experiments"}

packages = []
for name, folder in ROOTS.items():
    packages += [name, *(f"{name}.{sub}" for sub in find_packages(folder))]
data_packages = []
for name, folder in DATA_ROOTS.items():
    data_packages += [name, *(f"{name}.{sub}" for sub in find_namespace_packages(folder, exclude=["*__pycache__*"]))]

setup(
    package_dir={**ROOTS, **DATA_ROOTS},
    packages=packages + data_packages,
    package_data={"ecds_lab": ["py.typed"], **{name: ["*.yaml"] for name in data_packages}},
)
