; RobotHow (and RobotHow-Small, same action models with fewer objects): a household robot with
; two hands that walks, grabs, puts, opens, switches, plugs, wipes, washes and cuts.
;
; Object categories (grabbable, surface, container, ...) are static unary predicates. Which object
; may be put on or in which is decided by static "role" categories of the problem:
;   food, towel, towel_rack, dish_surface, dry_surface        (where Put is allowed)
;   food_in, cloth, dish, paper_item, kitchen_container, wardrobe, laundry, office, dish_machine
;                                                              (where PutIn is allowed)
; RobotHow-Small declares none of the PutIn roles, so there PutIn is allowed for every
; grabbable x container pair.
;
; Quirks kept on purpose (they are part of the published scenario):
;  * Putting the rag (a cleaning tool) down deletes IsHoldingCleaningTool(self) only: the hand is
;    "empty" and still holds the rag.
;  * Putting the knife down never deletes IsHoldingKnife(self).
;  * Cut(x) needs x in the LEFT hand; Wash(x) needs x in the RIGHT hand.
;  * PlugOut(x) needs IsSwitchedOff(x), also for objects without a switch.
;  * Both hands may grab the same object.
(define (domain robothow)
  (:requirements :strips :typing :equality :action-costs :disjunctive-preconditions :conditional-effects)
  (:constants self faucet)
  (:predicates
    (IsNear ?a ?x) (IsOn ?x ?y) (IsIn ?x ?y) (IsOpen ?x) (IsClose ?x) (IsSwitchedOn ?x) (IsSwitchedOff ?x)
    (IsPlugged ?x) (IsUnplugged ?x) (IsClean ?x) (IsCut ?x)
    (IsLeftHandEmpty ?a) (IsRightHandEmpty ?a) (IsLeftHolding ?a ?x) (IsRightHolding ?a ?x)
    (IsLeftHandFull ?a) (IsRightHandFull ?a) (IsHoldingCleaningTool ?a) (IsHoldingKnife ?a) (IsStanding ?a)
    (surface ?x) (sittable ?x) (can_open ?x) (container ?x) (grabbable ?x) (cleaning_tool ?x)
    (cutting_tool ?x) (has_switch ?x) (has_plug ?x) (eatable ?x) (cutable ?x) (washable ?x)
    (recipient ?x) (pourable ?x) (drinkable ?x) (all_objects ?x)
    (food ?x) (towel ?x) (towel_rack ?x) (dish_surface ?x) (dry_surface ?x)
    (food_in ?x) (cloth ?x) (dish ?x) (paper_item ?x)
    (kitchen_container ?x) (wardrobe ?x) (laundry ?x) (office ?x) (dish_machine ?x))
  (:functions (total-cost) - number)

  (:action Walk
    :parameters (?x)
    :precondition (and (all_objects ?x) (IsStanding self))
    :effect (and (IsNear self ?x)
                 (forall (?y) (when (and (all_objects ?y) (not (= ?y ?x))) (not (IsNear self ?y))))
                 (increase (total-cost) 15)))

  (:action RightGrab
    :parameters (?x)
    :precondition (and (grabbable ?x) (IsRightHandEmpty self) (IsNear self ?x))
    :effect (and (IsRightHolding self ?x) (IsRightHandFull self) (not (IsRightHandEmpty self))
                 (when (cleaning_tool ?x) (IsHoldingCleaningTool self))
                 (when (cutting_tool ?x) (IsHoldingKnife self))
                 (forall (?p) (when (surface ?p) (not (IsOn ?x ?p))))
                 (forall (?p) (when (container ?p) (not (IsIn ?x ?p))))
                 (increase (total-cost) 5)))

  (:action LeftGrab
    :parameters (?x)
    :precondition (and (grabbable ?x) (IsLeftHandEmpty self) (IsNear self ?x))
    :effect (and (IsLeftHolding self ?x) (IsLeftHandFull self) (not (IsLeftHandEmpty self))
                 (when (cleaning_tool ?x) (IsHoldingCleaningTool self))
                 (when (cutting_tool ?x) (IsHoldingKnife self))
                 (forall (?p) (when (surface ?p) (not (IsOn ?x ?p))))
                 (forall (?p) (when (container ?p) (not (IsIn ?x ?p))))
                 (increase (total-cost) 5)))

  ; Put: non-food on any surface but the towel rack and dish surfaces; food on any surface but
  ; the towel rack and dry surfaces; towels on the towel rack.
  (:action RightPut
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (surface ?y)
                       (or (and (not (towel_rack ?y))
                                (or (and (not (food ?x)) (not (dish_surface ?y)))
                                    (and (food ?x) (not (dry_surface ?y)))))
                           (and (towel ?x) (towel_rack ?y)))
                       (IsRightHolding self ?x) (IsNear self ?y))
    :effect (and (IsRightHandEmpty self) (IsOn ?x ?y)
                 (when (not (cleaning_tool ?x)) (not (IsRightHolding self ?x)))
                 (when (cleaning_tool ?x) (not (IsHoldingCleaningTool self)))
                 (increase (total-cost) 6)))

  (:action LeftPut
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (surface ?y)
                       (or (and (not (towel_rack ?y))
                                (or (and (not (food ?x)) (not (dish_surface ?y)))
                                    (and (food ?x) (not (dry_surface ?y)))))
                           (and (towel ?x) (towel_rack ?y)))
                       (IsLeftHolding self ?x) (IsNear self ?y))
    :effect (and (IsLeftHandEmpty self) (IsOn ?x ?y)
                 (when (not (cleaning_tool ?x)) (not (IsLeftHolding self ?x)))
                 (when (cleaning_tool ?x) (not (IsHoldingCleaningTool self)))
                 (increase (total-cost) 6)))

  ; PutIn: anything into a general container; food into kitchen containers; clothes into
  ; wardrobes and the laundry; paper into office containers; dishes into the dish machine.
  (:action RightPutIn
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (container ?y)
                       (or (and (not (kitchen_container ?y)) (not (wardrobe ?y)) (not (laundry ?y))
                                (not (office ?y)) (not (dish_machine ?y)))
                           (and (kitchen_container ?y) (food_in ?x))
                           (and (or (wardrobe ?y) (laundry ?y)) (cloth ?x))
                           (and (office ?y) (paper_item ?x))
                           (and (dish_machine ?y) (dish ?x)))
                       (IsRightHolding self ?x) (IsNear self ?y)
                       (imply (has_plug ?y) (IsPlugged ?y))
                       (imply (can_open ?y) (IsOpen ?y)))
    :effect (and (IsRightHandEmpty self) (IsIn ?x ?y)
                 (when (not (cleaning_tool ?x)) (not (IsRightHolding self ?x)))
                 (when (cleaning_tool ?x) (not (IsHoldingCleaningTool self)))
                 (increase (total-cost) 10)))

  (:action LeftPutIn
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (container ?y)
                       (or (and (not (kitchen_container ?y)) (not (wardrobe ?y)) (not (laundry ?y))
                                (not (office ?y)) (not (dish_machine ?y)))
                           (and (kitchen_container ?y) (food_in ?x))
                           (and (or (wardrobe ?y) (laundry ?y)) (cloth ?x))
                           (and (office ?y) (paper_item ?x))
                           (and (dish_machine ?y) (dish ?x)))
                       (IsLeftHolding self ?x) (IsNear self ?y)
                       (imply (has_plug ?y) (IsPlugged ?y))
                       (imply (can_open ?y) (IsOpen ?y)))
    :effect (and (IsLeftHandEmpty self) (IsIn ?x ?y)
                 (when (not (cleaning_tool ?x)) (not (IsLeftHolding self ?x)))
                 (when (cleaning_tool ?x) (not (IsHoldingCleaningTool self)))
                 (increase (total-cost) 10)))

  (:action Open
    :parameters (?x)
    :precondition (and (can_open ?x) (IsClose ?x) (IsNear self ?x) (IsLeftHandEmpty self)
                       (imply (has_switch ?x) (IsSwitchedOff ?x)))
    :effect (and (IsOpen ?x) (not (IsClose ?x)) (increase (total-cost) 3)))

  (:action Close
    :parameters (?x)
    :precondition (and (can_open ?x) (IsOpen ?x) (IsNear self ?x) (IsLeftHandEmpty self))
    :effect (and (IsClose ?x) (not (IsOpen ?x)) (increase (total-cost) 3)))

  (:action SwitchOn
    :parameters (?x)
    :precondition (and (has_switch ?x) (IsLeftHandEmpty self) (IsNear self ?x) (IsSwitchedOff ?x)
                       (imply (can_open ?x) (IsClose ?x))
                       (imply (has_plug ?x) (IsPlugged ?x)))
    :effect (and (IsSwitchedOn ?x) (not (IsSwitchedOff ?x)) (increase (total-cost) 8)))

  (:action SwitchOff
    :parameters (?x)
    :precondition (and (has_switch ?x) (IsLeftHandEmpty self) (IsNear self ?x) (IsSwitchedOn ?x))
    :effect (and (IsSwitchedOff ?x) (not (IsSwitchedOn ?x)) (increase (total-cost) 8)))

  (:action PlugIn
    :parameters (?x)
    :precondition (and (has_plug ?x) (IsLeftHandEmpty self) (IsNear self ?x) (IsUnplugged ?x))
    :effect (and (IsPlugged ?x) (not (IsUnplugged ?x)) (increase (total-cost) 8)))

  (:action PlugOut
    :parameters (?x)
    :precondition (and (has_plug ?x) (IsLeftHandEmpty self) (IsNear self ?x) (IsPlugged ?x) (IsSwitchedOff ?x))
    :effect (and (IsUnplugged ?x) (not (IsPlugged ?x)) (increase (total-cost) 8)))

  (:action Wipe
    :parameters (?x)
    :precondition (and (all_objects ?x) (not (eatable ?x)) (not (drinkable ?x)) (not (washable ?x))
                       (IsHoldingCleaningTool self) (IsNear self ?x))
    :effect (and (IsClean ?x) (increase (total-cost) 9)))

  (:action Wash
    :parameters (?x)
    :precondition (and (washable ?x) (IsRightHolding self ?x) (IsNear self faucet) (IsSwitchedOn faucet))
    :effect (and (IsClean ?x) (increase (total-cost) 9)))

  (:action Cut
    :parameters (?x)
    :precondition (and (cutable ?x) (IsHoldingKnife self) (IsLeftHolding self ?x))
    :effect (and (IsCut ?x) (increase (total-cost) 9)))
)
