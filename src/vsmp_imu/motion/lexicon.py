"""The lexicon: words of an SMP primitive (its name and description) -> anatomical movements.

`read_primitive(name, description)` returns a `Reading`: the movements of
`motion.anatomy` the words name (in the action part of the sentence), the
movements held meanwhile (after "while", "keeping", "with the", "holding"),
whether the primitive returns to where the body was (lower, return, back
to...), goes out and back within itself (... and back, back and forth), or
holds, the side it names (left / right limb) and the direction of a turn,
twist or side bend (+1 = to the left). Rules are regular expressions over the
lower-cased text with underscores read as spaces; every rule is listed in
`RULES` with the movement it gives, so docs/motion.md can print the table.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from vsmp_imu.motion.anatomy import MOVEMENTS

_ARM = r"(arms?|hands?|fists?|elbows?|forearms?|wrists?|dumbbells?|weights?|kettlebells?|bar|ball|racket|bat|club)"
_ANY = r"[a-z ,'-]*?"
# "draw the knees up" names the legs, not a hand drawn upward
_NOT_LEGS = r"(?!(the |both |each |one )?(left |right )?(knees?|legs?|thighs?|feet|foot)\b)"

# (pattern, movement): a movement is read when its pattern occurs in the action part
RULES: tuple[tuple[str, str], ...] = (
    # locomotion and whole-body movements
    (r"\b(walk|walks|walking|stroll|march(es|ing)? forward)\b|\bstep(s|ping)? forward onto the (left|right) heel"
     r"|\bland(s|ing)? on the (left|right) heel", "walk"),
    (r"\b(run|runs|running|jog|jogs|jogging|sprint\w*)\b|\bshort flight", "run"),
    (r"\b(upstairs|up the stairs|up a flight|next higher step|step(s|ping)? up|climb\w*)\b", "stairs_up"),
    (r"\b(downstairs|down the stairs|next lower step|step(s|ping)? down|descend\w* the stairs)\b", "stairs_down"),
    (r"\blunge|\bstep\w* forward " + _ANY + r"\b(lower|bend|descend)", "lunge"),
    (r"\b(squat\w*|crouch\w*)\b|\bbend\w* (the |both )?(hips and (the )?knees|knees and (the )?hips)"
     r"|\blower\w* the (body|hips)\b", "squat"),
    (r"\bbend\w* (the |both )?knees\b|\bknees? bend", "knee_bend"),
    (r"\b(jump\w*|hop|hops|hopping|leap\w*)\b|\bbounc\w*\b(?! (the |a )?(basket)?ball)", "jump"),
    (r"\bsit(s|ting)? (down|back|on (a|the) (chair|seat|bench|bed|sofa|couch))\b|\bonto the (seat|chair|bench|bed)"
     r"|\bseated posture|\bto sit\b|\bsit on the edge|\bedge of the (bed|chair)", "sit_down"),
    (r"\bsit(s|ting)? (down )?on the floor|\bsit on the ground", "sit_down_floor"),
    (r"\bsit(s|ting)? up\b|\b(rais|lift)\w* the trunk( and head)? (up )?(from|off)", "sit_down"),
    (r"\bstand(s|ing)? (back )?up\b|\bget(s|ting)? up\b|\brises?\b(?! onto)(?! on )|\bto standing\b"
     r"|\bextend\w* the hips and knees", "stand_up"),
    (r"\blie(s)? (down|flat|back)\b|\blying down\b|\blie(s)? (still )?on the back|\bflat on the back",
     "lie_down"),
    (r"\breclin\w*", "recline"),  # seated; from any other posture the compiler lies down
    (r"\bplank\b|\bpush[- ]?up position|\bon the hands and toes", "plank"),
    (r"\bface down\b|\bprone\b|\bon the (belly|stomach)\b", "lie_prone"),
    (r"\bkneel\w*", "kneel"),
    (r"\bturn(s|ing)? (the body |around|about)|\bturn(s|ing)? to (face|lie|sit|stand|the edge)\b|(?<!in )\bturn(s|ing)?(?=,|\.|$)|\bpivot\w*|(?<!trunk )(?<!torso )\bturn(s|ing)? (to the )?(left|right)\b"
     r"(?! ?(the )?(trunk|torso|chest|head|wheel|palm|hand|forearm|wrist))", "turn"),
    # trunk and neck
    (r"\bside bend|\bbend\w* (the (trunk|torso|body|upper body) )?(sideways|to the (left|right)( side)?|to (one|the) side)"
     r"|\blateral(ly)? flex|\blean\w* (the (trunk|torso|body) )?(sideways|to the (left|right)|to one side)"
     r"|\bshift the weight to one side|\btilt\w* the (trunk|torso)", "trunk_side_bend"),
    (r"\b(twist|rotat|turn)\w* (the |his |her )?(trunk|torso|upper body|shoulders|hips|chest|body)\b"
     r"|\btrunk (rotation|twist)|\btwist\w*|\bwoodchop|\b(trunk|torso|hips|shoulders) (turn|rotat|twist)\w*"
     r"|\bswing\w* (the )?(bat|racket|club|golf)|\bfollow\w* through|\bfinish\w* over"
     r"|\belbows? to the (opposite |left |right )?knees?\b", "trunk_rotation"),
    (r"\b(bend|lean|hinge|bow|tip|fold)\w* (the (trunk|torso|upper body|body|chest) )?(forward|over|down)\b"
     r"|\bbent (forward|over)|\bforward bend|\bgood morning|\btouch\w* the toes|\btoe touch|\bhinge\w*"
     r"|\bcurl\w* the trunk|\breach\w* (down )?to the (floor|ground|table)|\bpick\w* up", "trunk_flexion"),
    (r"\b(lean|arch|bend|tilt)\w* (the (trunk|torso|upper body|body) )?back(ward)?s?\b|\bback extension"
     , "trunk_extension"),
    (r"\bstraighten\w* (the )?(trunk|back|up)|\b(stand|sit)\w* (up )?(upright|straight|tall)", "trunk_upright"),
    (r"\bstraighten\w* (the |both )?legs|\bextend\w* (the |both )?(legs|knees)\b", "leg_straighten"),
    (r"\bnod\w*|\blook\w* down|\bchin (down|to the chest)|\bbow the head", "neck_flexion"),
    (r"\b(turn|rotat|shak)\w* the head|\blook\w* (to the )?(left|right|around|over the shoulder)", "neck_rotation"),
    # arms
    (r"\bcurl\w*\b(?! the trunk)(?! (the |both )?wrists?)|\bhammer|\bbend\w* (the |both |each |one )?(left |right )?(elbows?|arms?)"
     r"|\bflex\w* (the |both )?(left |right )?elbows?|\b(hands?|fists?|dumbbells?) (up )?to the shoulders?"
     r"|\bbeside the (left |right )?shoulders?|\bwith the elbows? bent|(?<!lower )(?<!drop )\bguard\b|\bpull\w* (it |them |the \w+ )?in\b|\bto the chest|\bover the chest"
     r"|\bbehind the head|\bbeside the head|\bin front of the (chest|chin|face)|\bpull\w* " + _NOT_LEGS + _ANY + r"\bup\b"
     r"|\brow\b|\brow(s|ing)\b|\bsteer\w*|\bwheel\b|\blift\w* (it|them)\b|\btoward the body"
     r"|\b(drink\w*|sip\w*|eat|eats|eating|bite)\b|\bto the (mouth|lips|face)\b|\bbrush\w* the teeth"
     r"|\b(comb|brush)\w* (the )?hair", "elbow_flexion"),  # daily living: the hand to the mouth or head
    (r"\bhands? on (the |his |her )?hips\b|\bakimbo\b", "hands_on_hips"),
    # held at the chest ("bring both palms together in front of the chest" is a clap, not a hold)
    (r"\bclasp\w* (the |both )?hands|\bhands? (clasped |together )(in front of|at) the chest\b"
     r"|\b(hands?|fists?) (up )?(to|at) the chest\b", "hands_at_chest"),
    (r"\bstraighten\w* (the |both |each )?(left |right )?(elbows?|arms?)|\bextend\w* (the |both |each |one )?"
     r"(left |right )?(elbows?|arms?|fists?|hands?)|\bpunch\w*|\bjab\w*|\bthrust\w*|\bpush\w* (forward|up|away|out)"
     r"|\barms? (straight|extended)|\bat full reach|\bslid\w* " + _NOT_LEGS + _ANY + r"\b(forward|away)\b|\bwhip\w*|\bthrow\w*|\brelease|\bdribbl\w*"
     r"|\bbounc\w* (the |a )?(basket)?ball", "elbow_extension"),
    (r"\bpunch\w*|\bjab\w*|\bstraight forward|\bwhip\w*|\bthrow\w*|\bwheel\b|\bsteer\w*|\b(rais|lift|reach|extend|hold|bring|push|swing|slide)\w* "
     + _NOT_LEGS + _ANY + r"\b(forward|in front|to the front)\b|\bfront raise|\bat chest height|\bchest height"
     r"|\bforward and up|\btoward the door|\bcatch\w* (the |a )?(\w+ )?ball\b", "shoulder_flexion"),
    # up the sides: a press overhead, a jumping jack (the arms rise in the plane the legs spread in)
    (r"\b(overhead|shoulder|military) press|\bpress\w* " + _NOT_LEGS + _ANY + r"\b(overhead|above the head)"
     r"|\bjumping jacks?\b|\bstar jumps?\b", "shoulder_abduction_overhead"),
    (r"\boverhead\b|\babove the head|\bup high|\breach\w* up\b|(?<!rope )\bover the head|\btoward the ceiling"
     r"|\bskyward|\bbehind the head|\boverhand|\bto the top\b|\bupper left|\bstraight up\b"
     r"|\b(draw|move|trace)\w* " + _NOT_LEGS + _ANY + r"\bup\b", "shoulder_flexion_overhead"),
    (r"\b(draw|move|trace)\w* " + _ANY + r"\bdown\b", "shoulder_flexion"),
    (r"\bout to the sides?\b|\bbeside the head|\b(rais|lift|spread|extend)\w* " + _NOT_LEGS + _ANY + r"\bto the sides?\b|\bsideways\b"
     r"|\blateral raise|\bspread\w* (the |both )?arms|\bout to the (left|right)"
     r"|\babduct\w*|\barms? (out|wide)\b|\b(rais|lift)\w* (the |both )?(left |right )?arms? out"
     r"|\b(comb|brush)\w* (the )?hair", "shoulder_abduction"),
    (r"\barms? (crossed|folded)\b|\b(cross|fold)\w* (them|the arms|both arms|the forearms)( over the chest)?\b",
     "arms_crossed"),
    (r"\bacross (the|his|her) (body|chest)|\bhug\w*"
     r"|\bswing\w* " + _ANY + r"\bto the left|\bsweep\w* " + _ANY + r"\b(across|inward|to the left)"
     r"|\bbring the hands together|\bhands together|\bpalms together|\bclap\w*|\bfly\b|\bflyes?\b"
     r"|\bforehand|\bacross\b|\b(draw|move|slide|trace|swipe)\w* " + _ANY + r"\bto the left", "shoulder_horizontal_adduction"),
    (r"\b(draw|pull|drive|row)\w* " + _ANY + r"\bback\b|\brow(s|ing)?\b|\bbackswing|\bwind\w* up\b|\bcock\w*"
     r"|\bswing\w* (the |both )?(left |right )?(arms?|bat|racket|club|hands?|ball) back\b|\belbows? back|\bto the waist|\btoward the waist|\bbehind the (body|shoulder)"
     r"|\btake\w* " + _ANY + r"\bback\b|\btoward the body", "shoulder_extension"),
    (r"\bsweep\w* " + _ANY + r"\b(out|outward|to the right|away)\b|\bopen\w* the arms|\breverse fly|\bout to the right"
     r"|\b(draw|move|slide|trace|swipe)\w* " + _ANY + r"\bto the right",
     "shoulder_horizontal_abduction"),
    (r"\bpull\w* (the |a )?(band|rope|cable|tube)s? apart|\bpull[- ]aparts?\b", "shoulder_horizontal_abduction"),
    (r"\binternal(ly)? rotat|\brotate\w* the (upper )?arms? in(ward)?\b", "shoulder_internal_rotation"),
    (r"\bexternal(ly)? rotat|\brotate\w* the (upper )?arms? out(ward)?\b", "shoulder_external_rotation"),
    (r"\bshrug\w*|\b(rais|lift|elevate)\w* the shoulders", "shoulder_elevation"),
    (r"\bpronat\w*|\bpalms? (facing |face |turned )?down|\bturn\w* the palms? down|\bknuckles up"
     r"|\b(rotate|turn|twist)\w* (the |both )?(left |right )?(forearms?|wrists?|hands?|doorknob|knob|key|screwdriver)\b"
     r"|\bforearm rotation", "forearm_pronation"),
    (r"\bsupinat\w*|\bpalms? (facing |face |turned )?up\b|\bturn\w* the palms? up", "forearm_supination"),
    (r"\bwrist curl|\bflex\w* the wrists?|\bwrists? flexed|\bcurl\w* the wrists?|\bsnap\w* the wrists?"
     r"|\bwrists? (swing|flick)|\bflick\w*|\btyp\w*|\bkeyboard|\bwrit(e|es|ing)\b", "wrist_flexion"),
    (r"\bextend\w* the wrists?|\breverse wrist curl|\bcock\w* the wrists?", "wrist_extension"),
    (r"(?<!of the )\bcircle\w*|\bcircular\b|\bcircumduct\w*|\bwindmill", "arm_circumduction"),
    (r"\bswing\w* (the |both |his |her )?(left |right )?arms?\b|\barms? swings?|\bpendulum|\bsweep\w* "
     + _ANY + r"\b(left|right) and back|\bwave\w*|\bsweep\w* the (cloth|hand)", "arm_pendulum_swing"),
    # legs
    (r"\b(lift|rais|drive|draw|pull|bring|tuck|swing|hug)\w* (the |both |each |one |the other )?(left |right )?(knees?|legs?|thighs?)\b"
     r"(?! (out|to the side|sideways|back|together|apart))|\bknee raise|\bhigh knees"
     r"|\bmarch\w*|\bleg raise|\bpedal|\b(elbow|hand)s? to the (opposite |left |right )?knees?\b"
     r"|\b(extend|straighten)\w* (the |both |each |one )?(left |right )?legs? (straight )?(forward|out in front|in front)\b",
     "hip_flexion"),
    (r"\bkick\w*", "leg_kick"),
    (r"\b(legs?|feet) apart|\bspread\w* (the |both )?legs|\bleg (out )?to the side|\bstep\w* (out )?to the side",
     "hip_abduction"),
    (r"\bon (the |his |her )?(toes|tiptoes?|balls of the feet)|\b(calf|heel) raise|\brise\w* onto|\bpush\w* off"
     r"|\blift\w* the heels|\bheels? (up|off)",
     "ankle_plantarflexion"),
)
_COMPILED = tuple((re.compile(p), m) for p, m in RULES)

RETURN_WORDS = re.compile(
    r"\b(lower|lowers|lowering|lowered|return|returns|returning|back to(?! the (left|right))|back down"
    r"|back inward|back overhead|relax\w*|uncross\w*|recover\w*|come back|comes back|drop|drops"
    r"|put \w+ (\w+ )?down|release it|let go|apart again|separate\w*)\b")
THERE_AND_BACK = re.compile(
    r"\band (back|return\w*|release\w*( it)?)\b(?! (the |a )?(ball|shot|throw|object))|\band (pull|bring|draw|push|put|step|swing|come|settle)"
    r"\w* (\w+ ){0,3}back\b|\bback and forth|\bto and fro|\bup and down|\band back\b"
    r"|\band (then )?(lower|drop|relax)\w* (it|them)\b")
HOLD_WORDS = re.compile(r"\b(hold|holds|holding|stay|stays|still|pause|pauses|remain\w*|rest)\b")
# the rest of the sentence describes a held posture ("keeping the arms extended", "while bent forward")
HELD_SPLIT = re.compile(r"\b(keeping|holding (the|both)|while (bent|seated|sitting|standing|lying|kneeling|bending))\b")
# the other limbs of gait ("while the right arm swings forward"): realized by the gait waves
OTHER_LIMB = re.compile(r"\bwhile the (left|right) (arm|leg|foot|hand)\b.*$")
# the place a movement starts from ("press the dumbbells from the shoulders to overhead")
FROM_PLACE = re.compile(r"\bfrom (?:the )?(shoulders?|chest|overhead|above the head|behind the head)\b")
# a posture named by a holding primitive or the first one
POSTURE_WORDS: tuple[tuple[str, str], ...] = (
    ("plank", r"\bplank\b|\bpush[- ]?up position|\bon the hands and toes"),
    ("lying_prone", r"\bface down\b|\bprone\b|\bon the (belly|stomach)\b"),
    ("lying", r"\b(lie|lies|lying)\b|\bon the back\b|\bsupine\b"),
    ("kneeling", r"\bkneel\w*"),
    ("sitting", r"\b(sit|sits|sitting|seated)\b"),
    ("standing", r"\b(stand|stands|standing)\b"),
)
# an arm raised or lifted with no direction: forward, when nothing else moves the shoulder
PLAIN_RAISE = re.compile(r"\b(rais|lift)\w* (the |both |each |one )?(left |right )?arms?\b")
# the pace the words set for one primitive, as a factor on its movements' durations at medium tempo:
# a strike, throw, kick or clap goes as fast as the speed limit lets the hand or foot go
BALLISTIC_WORDS = re.compile(
    r"\b(punch\w*|jab\w*|throw\w*|strike|strikes|striking|smash\w*|whip\w*|snap\w*|flick\w*|kick\w*|knock\w*"
    r"|toss\w*|slap\w*|spike\w*|clap\w*|uppercut\w*)\b|\brelease\w* (the |a )?(ball|shot|throw)"
    r"|\bswing\w* " + _NOT_LEGS + r"(the |both |his |her )?(\w+ ){0,2}(forward|through|down)\b")  # not "swing the arm back while ...", not a leg
QUICK_WORDS = re.compile(r"\b(quick|quickly|rapid|rapidly|fast|briskly|swift|swiftly|sharp|sharply|explosive\w*)\b")
SLOW_WORDS = re.compile(r"\b(slow|slowly|gently|gradually|carefully|steadily)\b")
PACE = {"ballistic": 0.3, "quick": 0.6, "slow": 1.5}
# knee lifts or steps that stay where they are: a gait that does not travel
IN_PLACE = re.compile(r"\b(in place|on the spot)\b")
_STEPPING = ("hip_flexion", "walk", "run")
# a curl turns the palms up as the elbows bend (a hammer curl keeps them facing each other)
CURL = re.compile(r"\bcurl(s|ing|ed)?\b")
HAMMER = re.compile(r"\bhammer\b|\bneutral grip|\bpalms? facing (each other|in(ward)?)\b")
GUARD_WORDS = re.compile(r"\b(punch\w*|jab\w*|box\w*|uppercut\w*|hook punch\w*)\b")
_LIMB_SIDE = re.compile(r"\b(left|right) (arm|hand|fist|elbow|forearm|wrist|shoulder|palm|leg|foot|knee|heel"
                        r"|thigh|hip|pedal|pole|toe)")
_DIRECTION = re.compile(r"\b(to the|toward the|towards the|over the) (left|right)\b|\b(left|right)ward"
                        r"|\bturn\w* (left|right)\b|\b(to|toward) the (left|right) (side|shoulder)")
_COUNTER = re.compile(r"\bcounter[- ]?clockwise|\banti[- ]?clockwise")
# limbs a primitive names: direction words ("forward", "out to the side") move the arms only when
# the words name no leg, or name an arm too
_LEG_WORDS = re.compile(r"\b(legs?|knees?|thighs?|feet|foot|heels?|toes?|ankles?|hips?|steps?|stepping)\b")
_ARM_WORDS = re.compile(r"\b(arms?|hands?|elbows?|fists?|wrists?|forearms?|shoulders?|palms?|fingers?"
                        r"|dumbbells?|kettlebells?|barbell|weights?|ball|racket|bat|club|poles?"
                        r"|punch\w*|jab\w*|uppercut\w*|throw\w*|clap\w*|wav\w*|box\w*|swim\w*|paddl\w*"
                        r"|hug\w*|drink\w*|sip\w*|eat|eats|eating|comb\w*|brush\w*|cup|glass|mug|spoon|fork)\b")
# movements that direction or place words alone can name ("the knee to the chest", a leg curl)
_DIRECTION_ONLY = ("shoulder_flexion", "shoulder_abduction", "shoulder_extension", "shoulder_horizontal_adduction",
                   "shoulder_horizontal_abduction", "elbow_flexion")
# the leg a person stands or balances on names the side that does not move
_SUPPORT = re.compile(r"\b(?:stand\w*|balanc\w*) on (?:the |one |his |her )?(left|right) (?:leg|foot)\b")
_LEG_PARTS = ("leg", "foot", "knee", "heel", "thigh", "hip", "pedal", "toe")



@dataclass(frozen=True)
class Reading:
    """What the lexicon reads in one primitive."""

    movements: tuple[str, ...]  # action movements, in rule order
    context: tuple[str, ...]  # movements held meanwhile ("while bent forward")
    returns: bool  # goes back to where the body was before the last outward primitive
    there_and_back: bool  # goes out and comes back within the primitive
    hold: bool  # names no movement: hold the current pose
    arm_side: str | None  # "left" / "right" when the words name one arm
    leg_side: str | None  # "left" / "right" when the words name one leg
    direction: int  # +1 left, -1 right, 0 unnamed (turns, twists, side bends, sweeps)
    counter_clockwise: bool
    posture: str | None  # the posture its words name (sit, lie, stand...), for holds and the start
    start: tuple[str, ...] = ()  # where the movement starts from ("press ... from the shoulders")
    pace: float = 1.0  # factor on the movements' durations: strikes and "quickly" shorten, "slowly" lengthens

    def all_movements(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(self.movements + self.context))


def normalize_text(text: str) -> str:
    """Lower case, underscores and hyphens as spaces, single spaces."""
    return re.sub(r"\s+", " ", re.sub(r"[_\-/]", " ", text.lower())).strip()


def movements_in(text: str) -> tuple[str, ...]:
    """Movements named anywhere in `text`, in rule order, redundant ones removed."""
    key = normalize_text(text)
    found = [m for rx, m in _COMPILED if rx.search(key)]
    return _prune(found)


def _prune(found: list[str]) -> tuple[str, ...]:
    out = list(dict.fromkeys(found))
    # a squat or lunge already bends the knees; running is not also walking
    if "squat" in out or "lunge" in out:
        out = [m for m in out if m != "knee_bend"]
    if any(m in out for m in ("run", "stairs_up", "stairs_down")):
        out = [m for m in out if m != "walk"]
    out = _overhead(out)
    if any(m in out for m in _PLACEMENTS):  # the hands' placement sets the arm: no other arm reach
        out = [m for m in out if m in _PLACEMENTS or m not in _REACHES]
    if "recline" in out:  # the trunk leans back with the pelvis
        out = [m for m in out if m not in ("trunk_flexion", "trunk_extension")]
    posture = [m for m in out if MOVEMENTS[m].kind == "posture"]
    if posture:
        # a change of support includes its own trunk and leg movements (and a recline before lying);
        # sitting down leans forward, so leaning back is a movement of its own ("sit on the bed and lean back")
        own = ("trunk_flexion", "knee_bend", "trunk_upright", "recline") + (
            () if posture == ["sit_down"] else ("trunk_extension",))
        out = [m for m in out if m not in own]
        keep = "plank" if "plank" in posture else posture[-1]  # face down on the hands and toes: a plank
        out = [m for m in out if MOVEMENTS[m].kind != "posture" or m == keep]
    return tuple(out)


_OVERHEAD = ("shoulder_flexion_overhead", "shoulder_abduction_overhead")
_PLACEMENTS = ("hands_on_hips", "hands_at_chest", "arms_crossed")
_REACHES = ("elbow_flexion", "shoulder_flexion", "shoulder_abduction", "shoulder_horizontal_adduction")


def _overhead(out: list[str]) -> list[str]:
    """Arms raised overhead, once: up the sides ("out to the sides and overhead", a press overhead, arms
    raised as the legs spread in a jumping jack) unless the words send them forward."""
    if not any(m in out for m in _OVERHEAD):
        return out
    sideways = "shoulder_abduction" in out or "hip_abduction" in out or (
        "shoulder_abduction_overhead" in out and "shoulder_flexion" not in out)
    up = "shoulder_abduction_overhead" if sideways else "shoulder_flexion_overhead"
    first = min(out.index(m) for m in _OVERHEAD if m in out)
    out = [up if i == first else m for i, m in enumerate(out)]
    return [m for i, m in enumerate(out) if i == first or m not in (
        *_OVERHEAD, "shoulder_flexion", "shoulder_abduction")]


def read_primitive(name: str, description: str = "", label: str = "") -> Reading:
    """The lexicon's reading of one primitive (its name and its description; the activity's label
    names the grip of a curl: a hammer curl)."""
    text = OTHER_LIMB.sub("", normalize_text(f"{name} . {description}"))
    action, context_text = _held_split(text, len(normalize_text(name)))
    back = THERE_AND_BACK.search(action)
    outward = action[:back.start()] if back else action
    action_moves = _ordered(FROM_PLACE.sub("", outward))  # where it starts from is not where it goes
    context = tuple(m for m in _ordered(context_text) if m not in action_moves
                    and MOVEMENTS[m].kind == "excursion")
    if GUARD_WORDS.search(text):
        context = (*context, "guard")  # punches start from and return to a guard
    if CURL.search(action) and "elbow_flexion" in action_moves and "forearm_supination" not in action_moves \
            and not HAMMER.search(f"{text} {normalize_text(label)}"):
        action_moves = (*action_moves, "forearm_supination")
    pace = _pace(action)
    action_moves = _in_place(text, action_moves, pace)
    returns = bool(RETURN_WORDS.search(action)) and not _outward_lowering(action, action_moves)
    there_back = bool(THERE_AND_BACK.search(text))
    if there_back and action_moves:
        returns = False
    hold = not action_moves and not returns
    arm_side, leg_side = _sides(action if action.strip(" .") else text)
    return Reading(action_moves, context, returns, there_back, hold, arm_side, leg_side,
                   _direction(action), bool(_COUNTER.search(text)), _posture(text), _start(outward, action_moves),
                   pace)


def _in_place(text: str, moves: tuple[str, ...], pace: float) -> tuple[str, ...]:
    """A knee lift or a step "in place": stepping in place, a jog in place when quick or running."""
    if not IN_PLACE.search(text) or not any(m in moves for m in _STEPPING):
        return moves
    gait = "jog_in_place" if pace < 1.0 or "run" in moves else "step_in_place"
    return (gait, *(m for m in moves if m not in _STEPPING))


def _pace(action: str) -> float:
    """The pace the action's words set (PACE): a strike or throw, quick, slow, else 1."""
    if BALLISTIC_WORDS.search(action):
        return PACE["ballistic"]
    if QUICK_WORDS.search(action):
        return PACE["quick"]
    return PACE["slow"] if SLOW_WORDS.search(action) else 1.0


def _held_split(text: str, name_len: int) -> tuple[str, str]:
    """(action, held): in the name and in the description each, the words from a held-posture phrase
    on ("keeping the arms extended") are held; a name that starts with one ("holding_the_bar") leaves
    the description its action."""
    action, held = [], []
    for part in (text[:name_len], text[name_len:]):
        hit = HELD_SPLIT.search(part)
        action.append(part[:hit.start()] if hit else part)
        held.append(part[hit.start():] if hit else "")
    return "".join(action), " . ".join(h for h in held if h)  # two phrases, as name and description are


def _ordered(text: str) -> tuple[str, ...]:
    """Movements in `text`; when both elbow movements match, the one named first wins; when both
    shoulder flexion and extension match, the one whose words end first ("swing the arm back while
    stepping forward": back); a swing back is not also a pendulum (which swings forward)."""
    found: list[tuple[int, int, str]] = []
    for rx, m in _COMPILED:
        hit = rx.search(text)
        if hit:
            found.append((hit.start(), hit.end(), m))
    names = [m for _, _, m in found]
    if "elbow_flexion" in names and "elbow_extension" in names:
        pos = {m: p for p, _, m in found}
        drop = "elbow_extension" if pos["elbow_flexion"] <= pos["elbow_extension"] else "elbow_flexion"
        names.remove(drop)
    if "shoulder_flexion" in names and "shoulder_extension" in names:
        end = {m: e for _, e, m in found}
        names.remove("shoulder_flexion" if end["shoulder_extension"] < end["shoulder_flexion"] else "shoulder_extension")
    if "arm_pendulum_swing" in names and "shoulder_extension" in names:
        names.remove("arm_pendulum_swing")  # a swing back is no pendulum forward
    names = list(_prune(names))
    if _LEG_WORDS.search(text) and not _ARM_WORDS.search(text):  # "swing the leg out to the side": no arm moves
        names = [m for m in names if m not in _DIRECTION_ONLY]
    if PLAIN_RAISE.search(text) and not any(MOVEMENTS[m].joint == "shoulder" for m in names):
        names.append("shoulder_flexion")  # an arm raised with no direction goes forward
    return tuple(names)


def _start(action: str, moves: tuple[str, ...]) -> tuple[str, ...]:
    """The placement a movement starts from: the hands at the shoulders or the chest, or overhead.
    A press overhead from the shoulders starts with the upper arms raised halfway in its plane
    and the elbows bent (the dumbbells at shoulder height)."""
    hit = FROM_PLACE.search(action)
    if not hit:
        return ()
    place = hit.group(1)
    # from the shoulders, a press starts with the upper arms halfway up its plane (the rack up the sides)
    halfway = {"shoulder_abduction_overhead": ("press_rack",),
               "shoulder_flexion_overhead": ("shoulder_flexion", "elbow_flexion")}
    rack = tuple(dict.fromkeys(m for raised in moves for m in halfway.get(raised, ()))) \
        if place.startswith("shoulder") else ()
    return rack or movements_in(f"hands to the {place}")


def _outward_lowering(action: str, moves: tuple[str, ...]) -> bool:
    """'lower the body into a squat', 'bend the elbows to lower the chest': lowering that goes out."""
    outward = {"squat", "knee_bend", "lunge", "elbow_flexion", "trunk_flexion", "sit_down", "sit_down_floor",
               "lie_down", "lie_prone", "kneel", "jump", "walk", "run", "stairs_down", "stairs_up"}
    if not any(m in outward for m in moves):
        return False
    return not re.search(r"\b(back (to|down|up|in)|again|return\w*)\b", action)


def _posture(text: str) -> str | None:
    for posture, pattern in POSTURE_WORDS:
        if re.search(pattern, text):
            return posture
    return None


def _sides(text: str) -> tuple[str | None, str | None]:
    support = _SUPPORT.search(text)
    if support:  # "standing on the left leg, lift the right leg": the leg that moves is the other one
        arm_side, leg_side = _sides(text[:support.start()] + text[support.end():])
        return arm_side, leg_side or ("right" if support.group(1) == "left" else "left")
    arm, leg = set(), set()
    for side, part in _LIMB_SIDE.findall(text):
        (leg if part in _LEG_PARTS else arm).add(side)
    # "... while the right arm swings forward": the side named first is the actor's
    first_arm = _first_side(text, leg=False)
    first_leg = _first_side(text, leg=True)
    return (first_arm if arm else None), (first_leg if leg else None)


def _first_side(text: str, leg: bool) -> str | None:
    for m in _LIMB_SIDE.finditer(text):
        if (m.group(2) in _LEG_PARTS) == leg:
            return m.group(1)
    return None


def _direction(text: str) -> int:
    m = _DIRECTION.search(text)
    if not m:
        return 0
    word = next(g for g in m.groups() if g in ("left", "right"))
    return 1 if word == "left" else -1


def lexicon_table() -> list[tuple[str, str]]:
    """(movement, pattern) rows for the docs."""
    return [(m, p) for p, m in RULES]
