"""scdp: Style-Conditioned Diffusion Policy, with the tasks, data, metrics and baselines to reproduce it.

Floor plan. The layers, bottom up; a module imports only from its own layer or below, and only at
module top (``tests/test_architecture.py`` reads this list and checks every import against it).
A module is imported by name (``importlib``) in five named places only, each to load what a run
may not need: the command's handler (cli), a user's ``module:OBJECT`` task (tasks), MuJoCo's GL
context at the first render (perception), diffusers' DPM-Solver at its first plan (policies),
Ray when a run asks for its executor (pipeline):

    robots       datasheet kinematics and limits of the Panda and the TurtleBot3
    envs         Gymnasium environments: the MuJoCo Panda, the differential drive
    tasks        the Task: dimensions, environment, kinematics, scene sampling, the bounds of a state
    perception   camera calibration, the simulated RGB-D camera, detection, location
    execution    Ruckig 1 kHz streaming, the Arm interface, the 1 ms simulated Panda
    data         scenes, Bezier demonstrations, the zarr replay buffer, training windows
    scoring      a scene's reference set; D, E, T of a path; the style subsets ranked by them
    models       the conditional U-Net (and its batch-1 speed path), scene encoder, style predictor
    policies     the Planner contract; DP, SCDP, Legibility Diffuser; checkpoints and load_method
    training     the one training loop and what each part learns from
    evaluation   rollouts, records, paired statistics, tables, claims, figures
    deploy       camera -> plan -> 1 kHz execution: one scene, many scenes, their pictures
    pipeline     ``scdp reproduce``: resumable stages, the executors that run them, the report
    serve        the HTTP planning service, and what the study's app shares with it: errors, body cap, socket
    study        the online observer study: stimuli, its web page and database, simulated participants, analysis
    cli          the ``scdp`` command

Leaves are the loose modules beside the layers: any layer may import them, and they import only
each other. They are:

    errors messages io keys planners sections config presets metrics observers ambiguity drawing threads devices content

A leaf that reads a task takes it through a small Protocol saying what it reads (tasks sit above the
leaves); so does an environment, which its task builds.
"""

__version__ = "0.1.0"

from scdp import threads as _threads

# No OpenGL choice here: importing scdp sets no MUJOCO_GL and imports no PyOpenGL, so commands
# that do not render run where no OpenGL library is installed; the renderer's context is chosen
# at the first render (scdp.perception.gl).

# Idle OpenMP threads sleep rather than spin, so scdp degrades gracefully beside other busy
# processes; set before torch is imported, and never over a user's choice (scdp.threads).
_threads.configure()
