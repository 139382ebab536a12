"""What the page asks besides the trials, and what it says at the end: the comprehension check
after the instructions, the confidence asked with every answer, the end-of-study ratings, and the
default debrief.

The comprehension check is scored by the server (:meth:`scdp.study.server.StudyServer.comprehend`);
the page receives the questions without their answers. A participant who fails it
:attr:`~scdp.study.record.StudyConfig.comprehension_attempts` times is screened out before any trial, with the study's screened-out code, as
participant platforms expect of a screening step. The ratings follow Dragan et al.'s subjective
measures: how early the goal was clear (legibility) and how much the motion was what one would
expect (predictability), each on a 7-point scale, asked of one motion per method the participant
saw, without naming the method.
"""

from __future__ import annotations

# (question, options, the index of the right option); the right option's place varies
COMPREHENSION = (
    ("When should you click a goal?",
     ("Only after the robot has stopped", "As soon as you think you know where the robot is going",
      "Before pressing Start")),
    ("You clicked a goal, then the robot seems to head elsewhere. What do you do?",
     ("Click the other goal: you can change your mind at any time", "Nothing: the first click is final",
      "Reload the page to see the motion again")),
    ("What happens if you reload the page while the robot moves?",
     ("The motion starts again from the beginning", "The trial is skipped",
      "The motion goes on from where it was: each motion plays once")),
)
ANSWERS = (1, 0, 2)

CONFIDENCE = ("a guess", "unsure", "fairly sure", "sure", "certain")  # 1..5, asked with every answer
SCALE = 7  # the ratings' points
RATINGS = {"legible": "From early in the motion, it was clear which goal the robot was heading to.",
           "predictable": "The robot moved the way I would have expected it to."}

DEFAULT_DEBRIEF = ("<p><b>Placeholder debrief.</b> The researcher running this study replaces it with the debrief "
                   "their ethics board approved, as <code>debrief.html</code> in the study folder (docs/study.md), "
                   "naming who to contact.</p><p>Thank you for taking part. The robot's motions were planned by "
                   "different methods: some move "
                   "directly, some exaggerate their motion early so that the goal is easier to tell apart. We measure "
                   "how early and how reliably people can tell where the robot is heading under each method. Some "
                   "trials also checked attention: where the motion ended, or an instruction at its end.</p>"
                   "<p>If you wish to withdraw your "
                   "answers, contact the researcher through the study platform's message system (or the contact "
                   "their debrief names) with your participant ID: they will be deleted.</p>")


def questions() -> list[dict]:
    """The comprehension check as the page receives it: questions and options, no answers."""
    return [{"question": q, "options": list(options)} for q, options in COMPREHENSION]


def comprehension_passed(answers: list[int]) -> bool:
    """Whether ``answers`` (one option index per question) are all right."""
    return list(answers) == list(ANSWERS)
